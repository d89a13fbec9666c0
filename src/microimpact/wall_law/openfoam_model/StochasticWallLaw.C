/*---------------------------------------------------------------------------*\
    microimpact -- a stochastic wall law as an OpenFOAM patch interaction model
    (see StochasticWallLaw.H). Written against OpenFOAM v1912's
    LocalInteraction and StandardWallInteraction.
\*---------------------------------------------------------------------------*/

#include "StochasticWallLaw.H"
#include "emptyPolyPatch.H"
#include "surfaceFilmRegionModel.H"

#include <cmath>

// * * * * * * * * * * * * * * Private Member Functions  * * * * * * * * * * //

template<class CloudType>
void Foam::StochasticWallLaw<CloudType>::readPatches()
{
    const dictionary& coeffs = this->coeffDict();
    const label n = entries_.size();
    kind_.setSize(n, label(pkNone));
    surface_.setSize(n, -1);
    captureEscapes_.setSize(n, false);
    e_.setSize(n, 1.0);
    mu_.setSize(n, 0.0);

    forAll(entries_, i)
    {
        const dictionary& d = entries_[i].dict;
        const keyType& name = entries_[i].patchName;
        const bool hasSurface = d.found("surface");
        const bool hasType = d.found("type");
        if (hasSurface == hasType)
        {
            FatalIOErrorInFunction(coeffs)
                << "patches entry " << name << " must have either `surface` "
                << "(a surface of the wall-law table, with `captured` stick or "
                << "escape) or `type` (localInteraction's none, rebound, stick "
                << "or escape), not " << (hasSurface ? "both" : "neither")
                << exit(FatalIOError);
        }
        if (hasSurface)
        {
            const string surface(d.get<string>("surface"));
            const int s = swl_surface_index(law_.get(), surface.c_str());
            if (s < 0)
            {
                wordList names(swl_size(law_.get(), SWL_DIM_SURFACE));
                forAll(names, j)
                {
                    names[j] = swl_surface_name(law_.get(), j);
                }
                FatalIOErrorInFunction(coeffs)
                    << "patches entry " << name << ": surface " << surface
                    << " is not in the table " << table_
                    << "; its surfaces are " << names << exit(FatalIOError);
            }
            const word captured(d.lookupOrDefault<word>("captured", "stick"));
            if (captured != "stick" && captured != "escape")
            {
                FatalIOErrorInFunction(coeffs)
                    << "patches entry " << name << ": captured " << captured
                    << " is not allowed; use stick or escape"
                    << exit(FatalIOError);
            }
            kind_[i] = pkWallLaw;
            surface_[i] = s;
            captureEscapes_[i] = (captured == "escape");
        }
        else
        {
            const word type(d.get<word>("type"));
            if (type == "none") kind_[i] = pkNone;
            else if (type == "rebound") kind_[i] = pkRebound;
            else if (type == "stick") kind_[i] = pkStick;
            else if (type == "escape") kind_[i] = pkEscape;
            else
            {
                FatalIOErrorInFunction(coeffs)
                    << "patches entry " << name << ": type " << type
                    << " is not allowed; use none, rebound, stick or escape, "
                    << "or give `surface` for a wall-law patch"
                    << exit(FatalIOError);
            }
            e_[i] = d.lookupOrDefault<scalar>("e", 1.0);
            mu_[i] = d.lookupOrDefault<scalar>("mu", 0.0);
        }
    }

    // The mesh's patches: the first matching entry wins
    const polyBoundaryMesh& bMesh = mesh_.boundaryMesh();
    patchToEntry_.setSize(bMesh.size(), -1);
    forAll(entries_, i)
    {
        const labelList ids(bMesh.indices(entries_[i].patchName));
        if (ids.empty())
        {
            WarningInFunction
                << "Cannot find any patch names matching "
                << entries_[i].patchName << endl;
        }
        for (const label id : ids)
        {
            if (patchToEntry_[id] < 0)
            {
                patchToEntry_[id] = i;
            }
        }
    }

    DynamicList<word> missing;
    forAll(bMesh, patchi)
    {
        const polyPatch& pp = bMesh[patchi];
        if
        (
            !pp.coupled()
         && !isA<emptyPolyPatch>(pp)
         && patchToEntry_[patchi] < 0
        )
        {
            missing.append(pp.name());
        }
    }
    if (missing.size())
    {
        FatalIOErrorInFunction(coeffs)
            << "stochasticWallLaw, like localInteraction, needs every "
            << "non-coupled, non-empty patch in `patches`. Add entries for "
            << "patches:" << nl << missing << nl
            << "(e.g. outlet { type escape; })" << exit(FatalIOError);
    }
}


template<class CloudType>
void Foam::StochasticWallLaw<CloudType>::checkFilm()
{
    if (filmChecked_)
    {
        return;
    }
    filmChecked_ = true;

    const word film
    (
        this->owner().subModelProperties().template
            lookupOrDefault<word>("surfaceFilmModel", "none")
    );
    typedef regionModels::surfaceFilmModels::surfaceFilmRegionModel filmType;
    const objectRegistry& db = mesh_.time();
    if (film == "none" || !db.foundObject<filmType>("surfaceFilmProperties"))
    {
        return;
    }
    const filmType& filmModel =
        db.lookupObject<filmType>("surfaceFilmProperties");

    DynamicList<word> lawPatches;
    DynamicList<word> otherPatches;
    forAll(patchToEntry_, patchi)
    {
        const label entryi = patchToEntry_[patchi];
        if (entryi < 0 || !filmModel.isRegionPatch(patchi))
        {
            continue;
        }
        const word& name = mesh_.boundaryMesh()[patchi].name();
        if (kind_[entryi] == pkWallLaw)
        {
            lawPatches.append(name);
        }
        else if (kind_[entryi] != pkNone)
        {
            otherPatches.append(name);
        }
    }
    if (otherPatches.size())
    {
        WarningInFunction
            << "the stochasticWallLaw entries of patches " << otherPatches
            << " of cloud " << this->owner().name() << " never act: the "
            << "surface film model " << film << " takes every parcel that "
            << "strikes them" << endl;
    }
    if (lawPatches.size())
    {
        FatalErrorInFunction
            << "patches " << lawPatches << " are wall-law patches of "
            << "stochasticWallLaw (cloud " << this->owner().name()
            << ") and patches of the surface film region (surfaceFilmModel "
            << film << "). OpenFOAM gives a parcel that strikes a film patch "
            << "to the film model, never to the patch interaction model, so "
            << "the wall law would not act there. Give these patches a "
            << "localInteraction entry in `patches` (e.g. { type rebound; }), "
            << "take them out of the film region, or set surfaceFilmModel none"
            << exit(FatalError);
    }
}


template<class CloudType>
void Foam::StochasticWallLaw<CloudType>::removeParcel
(
    typename CloudType::parcelType& p,
    const label entryi,
    const bool escape,
    bool& keepParticle
)
{
    const scalar dm = p.nParticle()*p.mass();
    p.active(false);
    p.U() = Zero;
    if (escape)
    {
        keepParticle = false;
        nEscape_[entryi]++;
        massEscape_[entryi] += dm;
    }
    else
    {
        keepParticle = true;
        nStick_[entryi]++;
        massStick_[entryi] += dm;
    }
    // a removed or stopped (inactive) parcel strikes no more: forget it
    struck_.erase(labelPair(p.origProc(), p.origId()));
}


template<class CloudType>
void Foam::StochasticWallLaw<CloudType>::pruneStruck()
{
    ++mark_;
    if (struck_.size())
    {
        for (const typename CloudType::parcelType& p : this->owner())
        {
            auto iter = struck_.find(labelPair(p.origProc(), p.origId()));
            if (iter.found())
            {
                *iter = mark_;
            }
        }
    }
    DynamicList<labelPair> gone;
    forAllConstIters(struck_, iter)
    {
        if (*iter != mark_)
        {
            gone.append(iter.key());
        }
    }
    for (const labelPair& key : gone)
    {
        struck_.erase(key);
    }

    if (Pstream::parRun())
    {
        // parcels that left another processor may be here now
        List<labelPairList> left(Pstream::nProcs());
        left[Pstream::myProcNo()] = gone;
        Pstream::gatherList(left);
        Pstream::scatterList(left);
        labelPairHashSet elsewhere;
        forAll(left, proci)
        {
            if (proci != Pstream::myProcNo())
            {
                elsewhere.insert(left[proci]);
            }
        }
        if (elsewhere.size())
        {
            for (const typename CloudType::parcelType& p : this->owner())
            {
                const labelPair key(p.origProc(), p.origId());
                if (elsewhere.found(key))
                {
                    struck_.set(key, mark_);
                }
            }
        }
    }
}


template<class CloudType>
Foam::label Foam::StochasticWallLaw<CloudType>::total
(
    const word& name,
    const label local
) const
{
    label stored = 0;
    this->getModelProperty(name, stored);
    return stored + returnReduce(local, sumOp<label>());
}


template<class CloudType>
Foam::labelList Foam::StochasticWallLaw<CloudType>::total
(
    const word& name,
    const labelList& local
) const
{
    labelList stored(local.size(), Zero);
    this->getModelProperty(name, stored);
    labelList sum(local);
    Pstream::listCombineGather(sum, plusEqOp<label>());
    Pstream::listCombineScatter(sum);
    forAll(sum, i)
    {
        sum[i] += (i < stored.size() ? stored[i] : 0);
    }
    return sum;
}


template<class CloudType>
Foam::scalarList Foam::StochasticWallLaw<CloudType>::total
(
    const word& name,
    const scalarList& local
) const
{
    scalarList stored(local.size(), Zero);
    this->getModelProperty(name, stored);
    scalarList sum(local);
    Pstream::listCombineGather(sum, plusEqOp<scalar>());
    Pstream::listCombineScatter(sum);
    forAll(sum, i)
    {
        sum[i] += (i < stored.size() ? stored[i] : 0);
    }
    return sum;
}


// * * * * * * * * * * * * Protected Member Functions  * * * * * * * * * * * //

template<class CloudType>
void Foam::StochasticWallLaw<CloudType>::writeFileHeader(Ostream& os)
{
    PatchInteractionModel<CloudType>::writeFileHeader(os);

    forAll(entries_, i)
    {
        const word name(entries_[i].patchName);
        this->writeTabbed(os, name + "_nEscape");
        this->writeTabbed(os, name + "_massEscape");
        this->writeTabbed(os, name + "_nStick");
        this->writeTabbed(os, name + "_massStick");
    }
    this->writeTabbed(os, "firstStrikes");
    this->writeTabbed(os, "capturedAtFirstStrike");
    this->writeTabbed(os, "strikes");
    this->writeTabbed(os, "reimpacts");
    this->writeTabbed(os, "forcedCaptures");
    this->writeTabbed(os, "clampedQueries");
}


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

template<class CloudType>
Foam::StochasticWallLaw<CloudType>::StochasticWallLaw
(
    const dictionary& dict,
    CloudType& cloud
)
:
    PatchInteractionModel<CloudType>(dict, cloud, typeName),
    mesh_(cloud.mesh()),
    table_(this->coeffDict().template get<fileName>("table")),
    law_(),
    entries_(this->coeffDict().lookup("patches")),
    kind_(),
    surface_(),
    captureEscapes_(),
    e_(),
    mu_(),
    patchToEntry_(),
    maxReimpacts_
    (
        this->coeffDict().template lookupOrDefault<label>("maxReimpacts", 10)
    ),
    warnClamped_(this->coeffDict().lookupOrDefault("warnClamped", true)),
    strictClamp_(this->coeffDict().lookupOrDefault("strictClamp", false)),
    warnedClamped_(false),
    nEscape_(entries_.size(), Zero),
    massEscape_(entries_.size(), Zero),
    nStick_(entries_.size(), Zero),
    massStick_(entries_.size(), Zero),
    nFirst_(0),
    nFirstCaptured_(0),
    nStrikes_(0),
    nReimpacts_(0),
    nForced_(0),
    nClamped_(0),
    struck_(),
    mark_(0),
    filmChecked_(false),
    resuspension_(this->coeffDict().lookupOrDefault("resuspension", false)),
    nResuspended_(0)
{
    const fileName given(table_);
    table_.expand();
    if (maxReimpacts_ < 0)
    {
        FatalIOErrorInFunction(this->coeffDict())
            << "maxReimpacts " << maxReimpacts_ << " must be >= 0"
            << exit(FatalIOError);
    }

    swl_law* raw = nullptr;
    const int rc = swl_load(table_.c_str(), &raw);
    if (rc != 0)
    {
        FatalIOErrorInFunction(this->coeffDict())
            << "cannot load the wall-law table " << table_
            << " (table " << given << "): " << swl_strerror(rc) << nl
            << "Copy microimpact's OUT/c/wall_law.swl there "
            << "(docs/wall-law.md)" << exit(FatalIOError);
    }
    law_.reset(raw, swl_free);
    if (resuspension_ && swl_has_stay(law_.get()) != 1)
    {
        FatalIOErrorInFunction(this->coeffDict())
            << "resuspension yes needs a table with stay_probability (built "
            << "with [resuspension]); " << table_ << " has none"
            << exit(FatalIOError);
    }

    readPatches();

    // the struck parcels of a restart (all processors' at the write)
    labelPairList stored;
    this->getModelProperty("struckParcels", stored);
    for (const labelPair& key : stored)
    {
        struck_.insert(key, 0);
    }
    if (stored.size())
    {
        Info<< "    stochasticWallLaw: " << stored.size() << " struck parcels "
            << "restored from the restart" << endl;
    }

    Info<< "    stochasticWallLaw: table " << table_ << " ("
        << swl_size(law_.get(), SWL_DIM_SURFACE) << " surfaces, "
        << swl_size(law_.get(), SWL_DIM_DIAMETER) << " x "
        << swl_size(law_.get(), SWL_DIM_SPEED)
        << (
               swl_speed_axis(law_.get()) == SWL_SPEED_REDUCED
             ? " reduced speeds v/v_c(d) x "
             : " x "
           )
        << swl_size(law_.get(), SWL_DIM_ANGLE) << " nodes, "
        << swl_size(law_.get(), SWL_DIM_RESERVOIR) << " rebounds per node)"
        << ", maxReimpacts " << maxReimpacts_
        << (strictClamp_ ? ", strictClamp yes" : "") << endl;
}


template<class CloudType>
Foam::StochasticWallLaw<CloudType>::StochasticWallLaw
(
    const StochasticWallLaw<CloudType>& pim
)
:
    PatchInteractionModel<CloudType>(pim),
    mesh_(pim.mesh_),
    table_(pim.table_),
    law_(pim.law_),
    entries_(pim.entries_),
    kind_(pim.kind_),
    surface_(pim.surface_),
    captureEscapes_(pim.captureEscapes_),
    e_(pim.e_),
    mu_(pim.mu_),
    patchToEntry_(pim.patchToEntry_),
    maxReimpacts_(pim.maxReimpacts_),
    warnClamped_(pim.warnClamped_),
    strictClamp_(pim.strictClamp_),
    warnedClamped_(pim.warnedClamped_),
    nEscape_(pim.nEscape_),
    massEscape_(pim.massEscape_),
    nStick_(pim.nStick_),
    massStick_(pim.massStick_),
    nFirst_(pim.nFirst_),
    nFirstCaptured_(pim.nFirstCaptured_),
    nStrikes_(pim.nStrikes_),
    nReimpacts_(pim.nReimpacts_),
    nForced_(pim.nForced_),
    nClamped_(pim.nClamped_),
    struck_(pim.struck_),
    mark_(pim.mark_),
    filmChecked_(pim.filmChecked_),
    resuspension_(pim.resuspension_),
    nResuspended_(pim.nResuspended_)
{}


// * * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * //

template<class CloudType>
bool Foam::StochasticWallLaw<CloudType>::correct
(
    typename CloudType::parcelType& p,
    const polyPatch& pp,
    bool& keepParticle
)
{
    checkFilm();

    const label patchi = pp.index();
    if (patchi < 0 || patchi >= patchToEntry_.size())
    {
        return false;
    }
    const label entryi = patchToEntry_[patchi];
    if (entryi < 0)
    {
        return false;
    }

    vector& U = p.U();

    switch (kind_[entryi])
    {
        case pkNone:
        {
            return false;
        }
        case pkEscape:
        {
            removeParcel(p, entryi, true, keepParticle);
            return true;
        }
        case pkStick:
        {
            removeParcel(p, entryi, false, keepParticle);
            return true;
        }
        case pkRebound:
        {
            // localInteraction's rebound (v1912 LocalInteraction.C)
            keepParticle = true;
            p.active(true);
            vector nw;
            vector Up;
            this->owner().patchData(p, pp, nw, Up);
            U -= Up;
            const scalar Un = U & nw;
            const vector Ut = U - Un*nw;
            if (Un > 0)
            {
                U -= (1.0 + e_[entryi])*Un*nw;
            }
            U -= mu_[entryi]*Ut;
            U += Up;
            return true;
        }
        default:
        break;
    }

    // The wall law
    keepParticle = true;
    p.active(true);

    vector nw;
    vector Up;
    this->owner().patchData(p, pp, nw, Up);
    const vector Urel(U - Up);
    if ((Urel & nw) <= 0)
    {
        // not moving into the wall (tracking round-off): leave it as it is
        return true;
    }

    const double diameterUm = p.d()*1e6;
    const double normal[3] = {-nw.x(), -nw.y(), -nw.z()};
    double vIn[3] = {Urel.x(), Urel.y(), Urel.z()};
    double vOut[3];

    const bool first = struck_.insert(labelPair(p.origProc(), p.origId()), 0);
    if (first)
    {
        nFirst_++;
    }
    nStrikes_++;

    Random& rnd = this->owner().rndGen();
    const double below1 = std::nextafter(1.0, 0.0);

    for (label reimpacts = 0; ; ++reimpacts)
    {
        double u[5];
        for (double& ui : u)
        {
            const double x = rnd.sample01<scalar>();
            ui = (x < 0.0 ? 0.0 : (x < 1.0 ? x : below1));
        }
        int flags = 0;
        const int rc = swl_rebound_velocity
        (
            law_.get(), surface_[entryi], diameterUm, vIn, normal, u, vOut,
            &flags
        );

        if ((flags & SWL_FLAG_CLAMPED) && strictClamp_)
        {
            const double speed =
                std::sqrt(vIn[0]*vIn[0] + vIn[1]*vIn[1] + vIn[2]*vIn[2]);
            const double vn = std::fabs
            (
                vIn[0]*normal[0] + vIn[1]*normal[1] + vIn[2]*normal[2]
            );
            const double angleDeg =
                speed > 0 ? std::asin(std::min(1.0, vn/speed))*180.0/M_PI : 0;
            FatalErrorInFunction
                << "strictClamp: a parcel of diameter " << diameterUm
                << " um at " << speed << " m/s, " << angleDeg
                << " deg from the wall, on patch " << pp.name()
                << " lies outside the table " << table_ << " ("
                << ((flags & SWL_FLAG_CLAMPED_DIAMETER) ? "diameter " : "")
                << ((flags & SWL_FLAG_CLAMPED_SPEED) ? "speed " : "")
                << ((flags & SWL_FLAG_CLAMPED_ANGLE) ? "angle " : "")
                << "outside its nodes); extend the table's nodes, or set "
                << "strictClamp no to use its end nodes" << exit(FatalError);
        }
        if (flags & SWL_FLAG_CLAMPED)
        {
            nClamped_++;
            if (warnClamped_ && !warnedClamped_)
            {
                warnedClamped_ = true;
                WarningInFunction
                    << "a parcel of diameter " << diameterUm << " um at "
                    << std::sqrt(vIn[0]*vIn[0] + vIn[1]*vIn[1] + vIn[2]*vIn[2])
                    << " m/s on patch " << pp.name()
                    << " lies outside the table " << table_
                    << " (flags " << flags << "): it uses the table's end "
                    << "nodes. Further clamped queries are counted in the "
                    << "stochasticWallLaw summary, not reported one by one."
                    << endl;
            }
        }

        if (rc == SWL_CAPTURED)
        {
            if (first && reimpacts == 0)
            {
                nFirstCaptured_++;
            }
            const bool gone = resuspension_ && (flags & SWL_FLAG_RESUSPENDED);
            nResuspended_ += gone;
            removeParcel
            (
                p, entryi, gone || captureEscapes_[entryi], keepParticle
            );
            return true;
        }
        if (rc == SWL_REBOUND)
        {
            if (flags & SWL_FLAG_REIMPACT)
            {
                if (reimpacts >= maxReimpacts_)
                {
                    nForced_++;
                    removeParcel
                    (
                        p, entryi, captureEscapes_[entryi], keepParticle
                    );
                    return true;
                }
                nReimpacts_++;
                for (int i = 0; i < 3; i++)
                {
                    vIn[i] = vOut[i];
                }
                continue;
            }
            U = Up + vector(vOut[0], vOut[1], vOut[2]);
            return true;
        }

        FatalErrorInFunction
            << "stochasticWallLaw on patch " << pp.name() << ": "
            << swl_strerror(rc) << " (code " << rc << ") for a parcel of "
            << "diameter " << diameterUm << " um, velocity ("
            << vIn[0] << ' ' << vIn[1] << ' ' << vIn[2]
            << ") relative to the wall, table " << table_
            << exit(FatalError);
    }

    return true;
}


template<class CloudType>
void Foam::StochasticWallLaw<CloudType>::info(Ostream& os)
{
    PatchInteractionModel<CloudType>::info(os);
    checkFilm();
    pruneStruck();

    const labelList npe(total("nEscape", nEscape_));
    const scalarList mpe(total("massEscape", massEscape_));
    const labelList nps(total("nStick", nStick_));
    const scalarList mps(total("massStick", massStick_));
    const label nFirst = total("firstStrikes", nFirst_);
    const label nFirstCaptured =
        total("capturedAtFirstStrike", nFirstCaptured_);
    const label nStrikes = total("strikes", nStrikes_);
    const label nReimpacts = total("reimpacts", nReimpacts_);
    const label nForced = total("forcedCaptures", nForced_);
    const label nClamped = total("clampedQueries", nClamped_);
    const label nResuspended = total("resuspended", nResuspended_);

    forAll(entries_, i)
    {
        os  << "    Parcel fate: patch (number, mass) "
            << entries_[i].patchName << nl
            << "      - escape                      = "
            << npe[i] << ", " << mpe[i] << nl
            << "      - stick                       = "
            << nps[i] << ", " << mps[i] << nl;

        this->file()
            << tab << npe[i] << tab << mpe[i]
            << tab << nps[i] << tab << mps[i];
    }

    os  << "    stochasticWallLaw: first strikes " << nFirst
        << ", captured at first strike " << nFirstCaptured << nl
        << "    stochasticWallLaw: strikes " << nStrikes
        << ", re-impacts " << nReimpacts
        << ", forced captures " << nForced
        << ", clamped queries " << nClamped << nl
        << "    stochasticWallLaw: struck parcels remembered "
        << returnReduce(struck_.size(), sumOp<label>())
        << " (in the cloud, not captured)" << nl;
    if (warnClamped_ && nClamped > 0)
    {
        os  << "    stochasticWallLaw: warning: " << nClamped
            << " queries lay outside the table and used its end nodes; "
            << "extend the table's nodes" << nl;
    }
    if (resuspension_)
    {
        os  << "    stochasticWallLaw: resuspended " << nResuspended
            << " of the captured parcels" << nl;
    }

    this->file()
        << tab << nFirst << tab << nFirstCaptured << tab << nStrikes
        << tab << nReimpacts << tab << nForced << tab << nClamped << endl;

    if (this->writeTime())
    {
        this->setModelProperty("nEscape", npe);
        this->setModelProperty("massEscape", mpe);
        this->setModelProperty("nStick", nps);
        this->setModelProperty("massStick", mps);
        this->setModelProperty("firstStrikes", nFirst);
        this->setModelProperty("capturedAtFirstStrike", nFirstCaptured);
        this->setModelProperty("strikes", nStrikes);
        this->setModelProperty("reimpacts", nReimpacts);
        this->setModelProperty("forcedCaptures", nForced);
        this->setModelProperty("clampedQueries", nClamped);
        this->setModelProperty("resuspended", nResuspended);

        // every processor's struck parcels, for a restart (the properties
        // are written by the master)
        List<labelPairList> keys(Pstream::nProcs());
        keys[Pstream::myProcNo()] = struck_.toc();
        Pstream::gatherList(keys);
        Pstream::scatterList(keys);
        labelPairList all;
        for (const labelPairList& k : keys)
        {
            all.append(k);
        }
        this->setModelProperty("struckParcels", all);

        nEscape_ = Zero;
        massEscape_ = Zero;
        nStick_ = Zero;
        massStick_ = Zero;
        nFirst_ = 0;
        nFirstCaptured_ = 0;
        nStrikes_ = 0;
        nReimpacts_ = 0;
        nForced_ = 0;
        nClamped_ = 0;
        nResuspended_ = 0;
    }
}
